"""Reading and writing motion files.

The names below load on first use (PEP 562 ``__getattr__``): ``import mocapkit.io`` reads no file format,
and the IMU readers' names come with OpenSim's ``.sto``/``.mot`` registered in ``READERS``.
"""

import importlib as _importlib

TYPE_CHECKING = False
if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and tests/import_graph.py
    from mocapkit.io.atomic import atomic_write_bytes, atomic_write_text, atomic_writer
    from mocapkit.io.imu.signals import (
        ACCEPTED_HEADERS,
        READERS,
        ColumnOptions,
        detect_format,
        format_row,
        load_signals,
        read_imu_csv,
        read_imu_file,
        read_imu_text,
        read_sensor_folder,
        register_reader,
        sample_data_path,
        write_signal_csv,
    )
    from mocapkit.io.loaders import (
        kind_of,
        load,
        load_markers,
        load_motion,
        write_markers,
    )
    from mocapkit.io.markers.wide_csv import read_markers_csv, write_markers_csv

#: module -> the names it gives the package on first use
_LAZY = {
    "mocapkit.io.atomic": ("atomic_write_bytes", "atomic_write_text", "atomic_writer"),
    "mocapkit.io.imu.signals": ("ACCEPTED_HEADERS", "READERS", "ColumnOptions", "detect_format", "format_row",
                                "load_signals", "read_imu_csv", "read_imu_file", "read_imu_text",
                                "read_sensor_folder", "register_reader", "sample_data_path", "write_signal_csv"),
    "mocapkit.io.loaders": ("kind_of", "load", "load_markers", "load_motion", "write_markers"),
    "mocapkit.io.markers.wide_csv": ("read_markers_csv", "write_markers_csv"),
}
_WHERE = {name: module for module, names in _LAZY.items() for name in names}


def __getattr__(name: str):
    """A name of ``__all__``, imported on first use and then kept."""
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    if _WHERE[name] == "mocapkit.io.imu.signals":
        from mocapkit.io.loaders import register_opensim_readers

        register_opensim_readers()
    value = getattr(_importlib.import_module(_WHERE[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = [
    "kind_of",
    "load",
    "load_markers",
    "load_motion",
    "read_markers_csv",
    "write_markers",
    "write_markers_csv",
    "ACCEPTED_HEADERS",
    "ColumnOptions",
    "READERS",
    "atomic_write_bytes",
    "atomic_write_text",
    "atomic_writer",
    "detect_format",
    "format_row",
    "load_signals",
    "read_imu_csv",
    "read_imu_file",
    "read_imu_text",
    "read_sensor_folder",
    "register_reader",
    "sample_data_path",
    "write_signal_csv",
]
