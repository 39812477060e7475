"""The rendering studies and reports."""
