# Rendering: sources added to raycastd_engine / engine_tests here.
