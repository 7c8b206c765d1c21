"""Single-object tracking (paper Sec. 3.3): the template search (``search``), Algorithm 1 before association
(``algorithm1``) and, after association, trajectories followed past their ends (``extend``)."""
