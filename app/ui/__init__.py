"""The imgui side: the panel, the timeline, the PC-pad widget and the imgui GL bridge."""
