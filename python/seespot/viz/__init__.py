"""Views of a live seespot trial: :mod:`seespot.viz.viser` (3-D, in viser)."""
