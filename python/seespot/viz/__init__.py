"""Views of seespot trials: :mod:`seespot.viz.viser` (a live session in 3-D, in
viser) and :mod:`seespot.viz.meshcat` (a trial as a standalone 3-D animation)."""
