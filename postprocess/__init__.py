"""Post-processing: wave measurement of recorded samples (analysis) and figures (plotting)."""
