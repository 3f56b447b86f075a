"""The SQLite results store and its pandas view (load_results).  Imports metrics (for its column
list), never the run or report packages."""
