"""Figures (matplotlib imported lazily; computation never imports this package)."""
