"""Planners on the mode-domain engine: the RHex flip and the snake climb."""
