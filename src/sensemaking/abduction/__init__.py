"""Per-frame abduction: gated facts by component (:mod:`.problem`), clingo (:mod:`.solver`),
the cache of its answers (:mod:`.components`)."""
