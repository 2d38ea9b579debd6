"""Measuring tools: ``gimbal-bench`` (speed, loss, same-data comparison), replay speed, and
the Allan tools' speed and round-trip checks."""
