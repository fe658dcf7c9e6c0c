"""The model: geometry (every k-space, range, wrap and resolution formula), the acquisition, the
image grid, window weights and the data types. Nothing here reads or writes a file."""
