# Kernels that execute the notebooks during the docs build: warnings only
# from the notebooks themselves. ipykernel 7 logs a warning about running
# over TCP without encryption at every start (the build talks to a kernel
# on the same machine through the loopback interface).
c = get_config()  # noqa: F821
c.IPKernelApp.log_level = "ERROR"
