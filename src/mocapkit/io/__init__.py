"""Reading and writing motion files."""

from mocapkit.io.atomic import atomic_write_bytes, atomic_write_text, atomic_writer
from mocapkit.io.imucsv import (
    ACCEPTED_HEADERS,
    READERS,
    detect_format,
    format_row,
    load_signals,
    read_imu_csv,
    read_imu_text,
    read_sensor_folder,
    register_reader,
    sample_data_path,
    write_signal_csv,
)

__all__ = [
    "ACCEPTED_HEADERS",
    "READERS",
    "atomic_write_bytes",
    "atomic_write_text",
    "atomic_writer",
    "detect_format",
    "format_row",
    "load_signals",
    "read_imu_csv",
    "read_imu_text",
    "read_sensor_folder",
    "register_reader",
    "sample_data_path",
    "write_signal_csv",
]
