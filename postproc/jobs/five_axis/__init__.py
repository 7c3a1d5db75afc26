"""Five-axis jobs: programs as tool paths, their work offsets, compensation, RTCP writers,
and the five-axis commands' library entry points."""
