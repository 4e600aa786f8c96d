"""Model stage: what a cloud is, before any light."""
