"""vadsim: simulator and diagnosis toolkit for vibration-assisted drilling tools."""
