"""From alignment to output: time map, merge, slerp sampling, finger transfer, finger sanity."""
