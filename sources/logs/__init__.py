"""Real robot logs as streams of laser scans, poses and sonar readings (see :mod:`evmap.sources.logs.scan`)."""
