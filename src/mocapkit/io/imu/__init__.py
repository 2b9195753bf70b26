"""IMU orientation exports read from their own header (CSV/text of any vendor, sensor folders, stdin)."""
