"""The ``sar`` command-line interface: thin click commands over the library."""
