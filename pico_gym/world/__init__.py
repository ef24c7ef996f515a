"""World geometry: maps, their loading and saving, the escape-room generator and grids."""
