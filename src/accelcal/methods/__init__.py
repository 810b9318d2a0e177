"""Test methods: simulate, reduce and identify, one module per method."""
