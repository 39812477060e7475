"""The models studies and reports."""
