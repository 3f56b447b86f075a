"""The source thesis: its printed tables (reference) and the search over its unknown
simulation details (search).  Imports metrics and the scene; the report imports it."""
