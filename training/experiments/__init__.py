"""Studies of ideas tried and not kept: each is a ``panolight dev`` tool (``TOOLS`` in training/commands.py, its only
registration) with its notebook in docs/studies/keylight_tried.md. Nothing shipped imports them.

- ``glare_law``: the glare law c E theta^-2 around compact clipped regions, and the gates that could trust it;
- ``regressors``: the per-source trees against small networks, region by region, out of fold;
- ``one_account``: a clear-sky sun that takes its region's whole decided energy (issue 46), scored by keylight-cv.
"""
