# -DRAYCASTD_SANITIZE=address,undefined builds everything with ASan+UBSan. UBSan is made fatal
# so a finding fails the test that triggered it instead of scrolling past in the log.
if(RAYCASTD_SANITIZE)
    add_compile_options(-fsanitize=${RAYCASTD_SANITIZE} -fno-omit-frame-pointer
                        -fno-sanitize-recover=all)
    add_link_options(-fsanitize=${RAYCASTD_SANITIZE})
endif()
# ThreadSanitizer cannot run the ifunc resolvers of multiversioned functions (they run before
# its runtime is up): such builds compile the default clone only (engine/geometry/target_clones.h).
if(RAYCASTD_SANITIZE MATCHES "thread")
    add_compile_definitions(RAYCASTD_NO_TARGET_CLONES)
endif()
