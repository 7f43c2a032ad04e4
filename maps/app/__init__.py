"""The application: the command line, runs of scenarios, their artefacts, figures and comparisons."""
