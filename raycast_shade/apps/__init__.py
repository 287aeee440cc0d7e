"""Front-ends on top of :func:`raycast_shade.render`: the command line, the
demo, animations and batch rendering."""
