"""exodigit command-line research tools (curves, draw, calibrate, plot, trial)."""
