"""The commands: what ``labcut.recommend_orientation``, ``labcut.evaluate_orientation``,
``labcut.render`` and the animations run. They check a request, ask the effect planner
(:mod:`labcut.planner`) and the time budgets, then answer with the layers below: the flash
problem and its scorer (:mod:`labcut.orientation`) and the renderer (:mod:`labcut.rendering`).
Nothing below this layer imports it (``tests/test_layers.py``)."""
