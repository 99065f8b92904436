"""Reports that recompute the reference paper's figures with the twin's models.

- :mod:`.command`: ``ballscrew-twin report paper|gaps`` (options, what each report runs);
- :mod:`.paper`: Figs. 9-11 of the paper (PNG + CSV);
- :mod:`.gaps`: the measured gaps against the paper (gaps.json), with :mod:`.dynamic_check`.
"""
