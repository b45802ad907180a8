"""Figures of squealkit results; matplotlib is imported only here, when a plot is asked for."""
