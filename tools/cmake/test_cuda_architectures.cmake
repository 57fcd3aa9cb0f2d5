# CTest CudaArchitecturesPick: dypho_pick_cuda_architectures against fake
# nvidia-smi programs (one reporting a GPU, one failing as it does without a
# driver or device) and an explicit request.
#   cmake -DWORK=<scratch dir> -P tools/cmake/test_cuda_architectures.cmake
include(${CMAKE_CURRENT_LIST_DIR}/DyphoCudaArchitectures.cmake)
file(MAKE_DIRECTORY ${WORK})
file(WRITE ${WORK}/smi_gpu "#!/bin/sh\necho 9.0\necho 9.0\n")
file(WRITE ${WORK}/smi_none "#!/bin/sh\necho 'NVIDIA-SMI has failed because it could not communicate with the NVIDIA driver.' >&2\nexit 9\n")
file(CHMOD ${WORK}/smi_gpu ${WORK}/smi_none PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE)

function(expect requested smi version want)
  dypho_pick_cuda_architectures(got "${requested}" "${smi}" "${version}")
  if(NOT got STREQUAL want)
    message(FATAL_ERROR "requested '${requested}', nvidia-smi '${smi}', CMake ${version}: got '${got}', want '${want}'")
  endif()
  message(STATUS "ok: '${requested}' / '${smi}' / ${version} -> ${got} (${got_REASON})")
endfunction()

expect(auto "${WORK}/smi_gpu" 3.25.1 "native")
expect(auto "${WORK}/smi_gpu" 3.22.0 "90")
expect(auto "${WORK}/smi_none" 3.25.1 "75-real;80-real;86-real;89-real;90")
expect(auto "" 3.25.1 "75-real;80-real;86-real;89-real;90")
expect("86" "${WORK}/smi_gpu" 3.25.1 "86")
expect("80;90" "" 3.25.1 "80;90")
