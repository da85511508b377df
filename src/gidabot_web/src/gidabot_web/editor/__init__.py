"""The building editor (``gidabot edit DIR``): a floor's map and blueprint in, a checked building out, in the
browser (docs/building-format.md, *With the editor*)."""
