"""Figures: each ``*_plot(result, ...)`` draws a computed result; matplotlib is imported lazily."""
