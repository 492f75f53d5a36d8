"""Figures; nothing below imports this package."""
