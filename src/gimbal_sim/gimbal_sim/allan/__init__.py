"""gimbal-allan: characterise a gyro or accelerometer from a bag (Allan deviation, IEEE Std 952 fit)."""
