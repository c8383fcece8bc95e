"""The accuracy report: what accuracy costs in time, measured in one run on this machine.

`python -m durer accuracy [--quick] [--output docs/accuracy.md]` renders and times

- anti-aliasing: every sampler at 1…256 samples per pixel against a 4096-spp stratified reference,
  on the showcase scene and an edge-heavy scene (2,000 small spheres), with each sampler's fitted
  convergence slope; plus adaptive sampling's target_error knob;
- precision: float vs double, time per ray and error (renders, and the numerics hard-case sweep);
- sphere method: algebraic vs geometric vs robust, time per ray and error as distance/radius grows
  (the sweep of `durer.reports.numerics`);
- effects: what diffuse light, shadows, specular, reflection and refraction each add in time;
- ambient occlusion: noise and time against AO samples per hit;
- presets: each of `durer.PRESETS`' time and error,

and writes the Markdown page with its tables and the PNG plots next to it (accuracy-*.png). Every
comparison is measured in the same run: timings are medians over rounds that each render every
configuration once (so the machine's drift hits all alike), from the core's own timer.
"""
