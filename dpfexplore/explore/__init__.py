"""The design-space explorer in the browser: a sweep dataset's tips on one map, verified designs.

``dpfexplore explore DATASET`` serves a local page (127.0.0.1 only) over one sweep dataset:

* :mod:`.data`: the dataset read once through the store's verified readers, as arrays; the
  page's filters (:class:`~.data.Filters`);
* :mod:`.raster`: the map's image, every kept row's tip binned into pixels on the server;
* :mod:`.designs`: a click or a typed target answered by the lookup's stages under the filters:
  nearest rows, refinement by the exact model, re-solve, and a design TOML read back;
* :mod:`.session`: one page's state and one method per gesture (no Bokeh);
* :mod:`.page`: the Bokeh document, a table of views (filters, map, designs);
* :mod:`.server`: the Bokeh server on the loopback interface, BokehJS served locally.

Bokeh is an optional dependency (``pip install dpfexplore[explore]``): only :mod:`.page` and
:mod:`.server` import it, when a page is served, so importing this package, :mod:`.data`,
:mod:`.raster`, :mod:`.designs` or :mod:`.session` does not.
"""
