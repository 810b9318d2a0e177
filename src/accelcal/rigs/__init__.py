"""Test rigs: what the accelerometer feels (inputs, sampling, noise)."""
