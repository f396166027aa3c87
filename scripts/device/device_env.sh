# Sourced by gpu_check.sh and volcanite_check.sh (from the repository root, with .devbundle/):
# the bundle's libraries and the machine's NVIDIA Vulkan driver, and the volumes both render.
b=${b:-$(pwd)/.devbundle}
export LD_LIBRARY_PATH=$b/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
for j in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /usr/share/vulkan/icd.d/nvidia_icd.json \
         /etc/vulkan/icd.d/nvidia_icd.json; do
    [ -f "$j" ] && { export VK_DRIVER_FILES=$j VK_ICD_FILENAMES=$j; break; }
done
# volume_of NAME CSGV: the .csgv to render for NAME (a number N: synth:N^3, written once with the
# csgv tool CSGV to /tmp/sN.csgv; else .devbundle/volumes/NAME.csgv), printed; status 1 when none.
volume_of() {
    if [ -f "$b/volumes/$1.csgv" ]; then echo "$b/volumes/$1.csgv"; return 0; fi
    [[ $1 =~ ^[0-9]+$ ]] || return 1
    [ -f "/tmp/s$1.csgv" ] || "$2" compress "synth:$1x$1x$1" "/tmp/s$1.csgv" --quiet >/dev/null || return 1
    echo "/tmp/s$1.csgv"
}
