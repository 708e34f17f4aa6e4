"""Figures drawn with matplotlib from stores and study results."""
