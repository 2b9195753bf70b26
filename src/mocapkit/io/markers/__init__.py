"""Marker and OpenSim files: C3D, Qualisys TSV, TRC/MOT/STO, Vicon Nexus CSV, the wide marker CSV."""
