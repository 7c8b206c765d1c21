"""Looking at a run: why two tracks were (not) linked (``explain``), the association graph as HTML or PNG
(``graph_view``), tracks drawn on the frames (``render``) and solvers side by side (``compare``)."""
