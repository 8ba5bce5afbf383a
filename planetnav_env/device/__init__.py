"""The batch core on a GPU: an episode bank drawn on the host, and a vector env whose state stays on the
device (torch tensors, stepped by the CUDA entry points of :mod:`planetnav_env.core.cuda_entry`).

* :mod:`planetnav_env.device.bank`: :class:`~planetnav_env.device.bank.EpisodeBank`, the host-side part of
  ``M`` resets drawn in advance by :meth:`BatchCore.draw_row <planetnav_env.batch.BatchCore.draw_row>`
  (the CPU reset's own code), laid out like the state's rows, in the CPU vector env's order of episodes;
* :mod:`planetnav_env.device.refill`: :class:`~planetnav_env.device.refill.BankRefill`, the bank's next
  passes drawn on a host thread while the rows step, written into the slots the rows have left;
* :mod:`planetnav_env.device.draw_pool`: :class:`~planetnav_env.device.draw_pool.DrawPool`, processes that
  draw the bank's episodes in parallel, each for its own rows;
* :mod:`planetnav_env.device.rows`: the autoreset thread function (copy a bank row into a state row, then
  the compiled reset), and the row loops that run the thread functions on the CPU;
* :mod:`planetnav_env.device.vector_env`: :class:`~planetnav_env.device.vector_env.DeviceVectorEnv`;
* :mod:`planetnav_env.device.cuda_kernels`: the autoreset kernel, and the process's one dispatcher of each
  kernel;
* :mod:`planetnav_env.device.kernel_resources` and :mod:`planetnav_env.device.occupancy`: what the kernels
  cost a multiprocessor (registers, spills, from ``ptxas`` without a GPU) and the occupancy that allows;
* :mod:`planetnav_env.device.parity`: the GPU-against-CPU comparison, its stated tolerance and the
  recorded runs it compares;
* :mod:`planetnav_env.device.preflight`: the device check's first minute, a chain of checks that the
  machine's CUDA stack runs the device env at all (host mode standing in on the CPU).

Nothing here imports torch or numba-cuda at import time of the package: the modules that need them import
them themselves (torch comes with the ``[train]`` and ``[gpu]`` extras, numba-cuda with ``[gpu]``).
"""
