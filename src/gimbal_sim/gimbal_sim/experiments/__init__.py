"""The paper runners: one-process experiments that drive the cores of gimbal_estimators and
gimbal_control with gimbal_sim's world models (no ROS), each with its own command line,
``python -m gimbal_sim.experiments.<name> --help``. Their Monte Carlo campaigns run on the
campaign engine (:mod:`gimbal_sim.campaign`); :mod:`.registry` lists them.
"""
