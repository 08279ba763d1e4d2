"""HDF5 input/output. Names: :mod:`granwave.io.schema`; files: :mod:`granwave.io.files`."""

from .files import (check_writable, file_schema, read_linear, read_modes, read_packing,
                    read_signal, write_linear, write_modes, write_packing, write_signal)

__all__ = ["check_writable", "file_schema", "read_linear", "read_modes", "read_packing",
           "read_signal", "write_linear", "write_modes", "write_packing", "write_signal"]
