"""File formats: schemas, readers with validation, writers that write atomically."""
