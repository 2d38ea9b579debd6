"""The command-line edge: the one error boundary every console command runs inside
(``boundary``) and the ``gimbal-geometry`` command over the maths room (``geometry``)."""
