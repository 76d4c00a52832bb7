"""The per-cycle whole-body QP: tasks (costs), limits (constraints), solvers, the IK step."""
