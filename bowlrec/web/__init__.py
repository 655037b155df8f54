"""The web app of ``bowlrec serve``: HTML pages, figures and the offline rerun web viewer."""
