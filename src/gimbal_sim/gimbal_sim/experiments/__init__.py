"""Experiment runners (Monte Carlo tables), each ``python -m gimbal_sim.experiments.<name>``."""
