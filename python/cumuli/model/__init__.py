"""Model stage: cloud data and generators."""
