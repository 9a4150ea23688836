"""What the chapters use to show results: plotting, tables (``reporting``), the chapters'
parameter loading and checks (``chapter``), the downloadable datasets and the animations.

Imports every layer below it; nothing in the library imports it.
"""
