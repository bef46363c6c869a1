"""Property tests draw their examples deterministically.

Every run, on any machine, checks the same random systems (hypothesis'
``derandomize``: examples derived from each test's name), so a failure is
reproducible from the test's name alone and a green run is never a matter
of which examples came up. No deadline: a loaded machine runs slower, and
no test may depend on its speed.
"""

from hypothesis import settings

settings.register_profile("control_ncs", derandomize=True, deadline=None)
settings.load_profile("control_ncs")
