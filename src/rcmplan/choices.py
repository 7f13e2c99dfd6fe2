"""The names a scenario file and the command line choose among, in a module that imports
nothing: the command line lists them as it starts without importing the numerical stack that
builds each, and the modules that build them check a name against these lists.

- METHODS: the control methods (`--method`, `[controller] method`), built by
  `rcmplan.control.methods.make_solver`; DEFAULT_METHOD when a scenario names none;
  CURVED_METHODS those a curved needle runs (its solvers have no thesis variant).
- PLANTS: the plants (`--plant`, `plant`), built by `rcmplan.sim.registry.make_plant` (a test
  checks that its table has exactly these).
"""

METHODS = ("pinv", "pinv-thesis", "dls", "qp")
DEFAULT_METHOD = "pinv"
CURVED_METHODS = ("pinv", "dls", "qp")
PLANTS = ("kinematic", "mujoco", "mujoco-kinematic")
