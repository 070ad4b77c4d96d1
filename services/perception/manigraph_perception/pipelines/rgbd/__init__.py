"""Objects from an RGB-D camera, without markers: table plane, segmentation, pose, size and
colour, identity over time (docs/perception.md, "RGB-D")."""
