"""The floor: the plan (rooms, walls, doors, furniture), its drawing as map_server's map, and
the occupancy grid loaded back from that map."""
