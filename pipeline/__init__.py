"""signcast command line, orchestration, scenarios and progress."""
