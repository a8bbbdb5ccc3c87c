"""The gallery's image scraper for the figures spherekin.plot returns.

spherekin.plot's functions build a ``matplotlib.figure.Figure`` directly (no pyplot: a script, a
notebook or a server gets the figure without a GUI backend), so sphinx-gallery's matplotlib scraper,
which asks pyplot for its open figures, does not see them. This scraper saves every Figure that an
example's globals hold and pyplot does not manage, once per example, after the block that made it. It
runs before the matplotlib scraper (docs/conf.py), which closes pyplot's figures: run after it, a
pyplot figure held in a variable would look unmanaged and be saved twice.
"""

from __future__ import annotations

SEEN_KEY = "spherekin_scraped_figures"   # ids of the Figures already saved, kept in the example's vars


def scrape_figures(block, block_vars, gallery_conf):
    """The reST of the unmanaged Figures new in the example's globals after ``block`` ("" if none)."""
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure
    from sphinx_gallery.scrapers import figure_rst

    managed = {id(plt.figure(n)) for n in plt.get_fignums()}
    seen = block_vars.setdefault(SEEN_KEY, set())
    paths = []
    for value in list(block_vars["fake_main"].__dict__.values()):
        if isinstance(value, Figure) and id(value) not in managed and id(value) not in seen:
            seen.add(id(value))
            path = next(block_vars["image_path_iterator"])
            value.savefig(path)
            paths.append(path)
    return figure_rst(paths, gallery_conf["src_dir"])
