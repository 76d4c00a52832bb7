"""Motion generation: geometric paths timed by one Ruckig-driven path parameter."""
