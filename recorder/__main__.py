from recorder.command import main

main()
