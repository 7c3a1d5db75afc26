"""Jobs on program files: compensate a program, a stream of it, a batch of programs; subdivide;
convert's configuration data. The one floor where programs (languages) and compensation meet."""
