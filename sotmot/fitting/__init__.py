"""What the fit scripts share: labelling a run against ground truth and fitting the confidence maps and the
confirmation model (``confidence``), the lifted solver's pair costs (``lifted``)."""
