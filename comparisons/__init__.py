"""The shared encoder layer: video objects, shapes, FBA/BBA and motion coders, entropy coders, metrics, reports."""
