"""The masks studies and reports."""
