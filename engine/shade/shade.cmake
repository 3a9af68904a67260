# Shading (Phong, Whitted ray trees): sources added by engine/shade/shade.cmake.
