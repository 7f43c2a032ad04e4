"""The simulator: worlds, scenario files, the world generator and the sensors' world models.

Everything here stands for the real world and its physics. The evidence side
(``evmap.sources``) and the map (``evmap.maps``) read what these models measure,
never the world's ground truth, which only the evaluation reads.
"""
