"""The rig: skeleton roles, up axis, handedness, hand geometry, dropout repair, virtual and optical markers."""
