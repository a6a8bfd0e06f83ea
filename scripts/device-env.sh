# Sourced by the device-machine scripts: unpacks the Vulkan loader staged in .gl (by
# ../shared/tools/device-prep.sh) and points the loader at NVIDIA's ICD when it is there.
if ls .gl/*.deb >/dev/null 2>&1; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
if [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
