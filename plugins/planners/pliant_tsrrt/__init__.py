"""TS-RRT (Scholz & Stilman, poster ICHR 2010): push models of unfamiliar objects, object-space planning toward the
cheapest arrangement, execution with monitoring and replanning.  The planner ``tsrrt`` and the learner
``push-models`` share this package (the primitives, the models and their file format)."""
