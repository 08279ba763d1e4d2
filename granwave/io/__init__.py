"""HDF5 input/output. Names: :mod:`granwave.io.schema`; files: :mod:`granwave.io.files`.

The readers and writers are loaded on first use so that ``granwave.model``
can import the schema constants without an import cycle (model -> io.schema,
io.files -> model).
"""

_FILE_FUNCTIONS = ("check_writable", "file_schema", "read_linear", "read_modes", "read_packing",
                   "read_signal", "write_linear", "write_modes", "write_packing", "write_signal")

__all__ = list(_FILE_FUNCTIONS)


def __getattr__(name):
    if name in _FILE_FUNCTIONS:
        from . import files
        return getattr(files, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
