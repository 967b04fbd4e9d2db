"""Per-frame abduction: numpy gating into facts (:mod:`.problem`), clingo solving (:mod:`.solver`)."""
