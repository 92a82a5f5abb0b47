"""Applications built on the framework: they use problems, optimizers and the runner, and the
framework knows nothing of them.

- :mod:`metaknot.apps.fit`: ``metaknot fit``, a user's points to the fewest control points
  within a tolerance (also :func:`metaknot.fit`);
- :mod:`metaknot.apps.fit_output`: the files a fit writes;
- :mod:`metaknot.apps.commands`: the ``fit`` and ``demo`` commands of the ``metaknot`` command
  line.
"""
