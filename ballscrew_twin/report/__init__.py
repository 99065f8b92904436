"""Reports that recompute the reference paper's figures with the twin's models.

- :mod:`.paper`: ``ballscrew-twin report paper``, Figs. 9-11 of the paper (PNG + CSV).
"""
