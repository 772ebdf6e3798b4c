"""Command-line front end of labcut (console script ``labcut``)."""
