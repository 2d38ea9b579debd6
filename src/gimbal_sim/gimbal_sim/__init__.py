"""Simulation of host vehicles, gimbal dynamics and sensors in deterministic lockstep; MCAP recording, bag tools and the scenario orchestrator."""
