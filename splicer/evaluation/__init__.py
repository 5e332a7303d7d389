"""Ground-truth evaluation and synthetic data (never imported by the runtime)."""
