"""Recordings, fits and diagnoses, shared by the explorer's session and the file-based runs."""
