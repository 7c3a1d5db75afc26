"""The machining process: cutting forces, tool engagement, the workpiece's placement."""
