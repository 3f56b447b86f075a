"""Speech enhancers for scenesim and their plugin registry."""
