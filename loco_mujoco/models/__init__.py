"""Robot models: where they come from and how we edit them before compiling."""
