"""Reading and writing motion files."""

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

from mocapkit.io.loaders import kind_of, load, load_markers, load_motion, write_markers  # also registers .sto/.mot
from mocapkit.io.markers.wide_csv import read_markers_csv, write_markers_csv

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
