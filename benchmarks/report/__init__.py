"""Reports from a results store: tables, figures, the HTML listening page, store comparisons and
the thesis' reference tables.  Imports the store, metrics and run packages; nothing below imports it."""
