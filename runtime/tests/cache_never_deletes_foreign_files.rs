//! The cache removes stale staging folders of dead runs, and only those: pointed at a
//! folder that holds other things it refuses the folder, and inside a cache it
//! touches only the names it makes.

use objectsplat_runtime::store::Store;

#[test]
fn a_lock_file_and_its_sibling_folder_inside_the_cache_are_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    drop(Store::open(&cache).unwrap());
    // Someone else's `project.lock` with its `project/` folder, in the staging area.
    let tmp = cache.join("tmp");
    std::fs::write(tmp.join("project.lock"), "").unwrap();
    std::fs::create_dir(tmp.join("project")).unwrap();
    std::fs::write(tmp.join("project/notes.txt"), "keep me").unwrap();
    // And a staging folder of a dead run, which must go.
    std::fs::write(tmp.join("4242-17.lock"), "").unwrap();
    std::fs::create_dir(tmp.join("4242-17")).unwrap();

    drop(Store::open(&cache).unwrap());
    assert_eq!(
        std::fs::read_to_string(tmp.join("project/notes.txt")).unwrap(),
        "keep me"
    );
    assert!(tmp.join("project.lock").exists());
    assert!(!tmp.join("4242-17").exists() && !tmp.join("4242-17.lock").exists());
}

#[test]
fn a_folder_holding_other_files_is_not_adopted_as_a_cache() {
    let dir = tempfile::tempdir().unwrap();
    let project = dir.path().join("project");
    std::fs::create_dir_all(project.join("tmp/work")).unwrap();
    std::fs::write(project.join("project.lock"), "").unwrap();
    std::fs::write(project.join("tmp/work.lock"), "").unwrap();
    std::fs::write(project.join("tmp/work/data.txt"), "keep me").unwrap();

    let e = Store::open(&project).err().expect("refused").to_string();
    assert!(e.contains("not an objectsplat cache"), "{e}");
    assert_eq!(
        std::fs::read_to_string(project.join("tmp/work/data.txt")).unwrap(),
        "keep me"
    );
    assert!(!project.join("blobs").exists(), "nothing was created");
    // An empty folder, or a cache made earlier, is fine.
    std::fs::create_dir(dir.path().join("empty")).unwrap();
    assert!(Store::open(&dir.path().join("empty")).is_ok());
    assert!(Store::open(&dir.path().join("empty")).is_ok());
}
