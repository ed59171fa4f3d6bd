"""Studies of ideas tried and not kept: each is a ``panolight dev`` tool (``TOOLS`` in training/commands.py, its only
registration) with its notebook in docs/studies/keylight_tried.md. Nothing shipped imports them.

- ``glare_law``: the glare law c E theta^-2 around compact clipped regions, and the gates that could trust it;
- ``regressors``: the per-source trees against small networks, region by region, out of fold;
- ``key_variants``: what a key light carries (one account of its region's energy, a sure sun at its belief; issue 46),
  scored by keylight-cv;
- ``energy_oracle``, ``restore_harm``: a restored HDR's key light at the truth's energy, and what restoring does to
  every scene, with a dominant source or none (issue 45; docs/studies/captures.md);
- ``bracket_merge``: the merge's dark-ring rule and camera-curve gain against the rules they replaced (shipped; the
  evidence in docs/studies/captures.md).
"""
