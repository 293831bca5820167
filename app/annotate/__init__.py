"""``seedtrack annotate``: make and fix ground truth by pointing, in a local web page."""
