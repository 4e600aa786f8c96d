"""File formats that know nothing of clouds: images (`images`) and meshes (`meshes`)."""
