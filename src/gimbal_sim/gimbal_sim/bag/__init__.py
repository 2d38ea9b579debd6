"""rosbag2-compatible MCAP bags: schemas, writer, reader/recovery, recorder and player."""
