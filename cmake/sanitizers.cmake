# -DRAYCASTD_SANITIZE=address,undefined builds everything with ASan+UBSan. UBSan is made fatal
# so a finding fails the test that triggered it instead of scrolling past in the log.
if(RAYCASTD_SANITIZE)
    add_compile_options(-fsanitize=${RAYCASTD_SANITIZE} -fno-omit-frame-pointer
                        -fno-sanitize-recover=all)
    add_link_options(-fsanitize=${RAYCASTD_SANITIZE})
endif()
