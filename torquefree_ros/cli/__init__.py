"""The console scripts, one module each (``torquefree_sim``, ``torquefree_bag``, ...): argument
parsing, help and process manners only; the work is done by ``core``, ``bag`` and ``ros``."""
