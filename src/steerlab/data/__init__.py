"""Recordings, readers, preprocessing, modalities, the compiled cache and splits."""
