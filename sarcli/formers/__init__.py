"""Image-former kernels: pure array-in/array-out functions that ``sarcli.formation`` wires up.

- :mod:`.direct`: the exact matched filter (eq. ``mf``), far-field and spherical, the reference.
- :mod:`.nufft`: the far-field matched filter as one type-1 NUFFT (FINUFFT).
- :mod:`.pfa`: the polar format algorithm (gridding onto a Cartesian k-grid, then FFT).
"""
