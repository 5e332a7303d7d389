"""The alignment: frame spaces, bands, the DTW engine (open ends), the two metrics, the passes, the expected path, confidence."""
