"""`wbpower simulate -o DIR` (see shared/spec/cli.md)."""
